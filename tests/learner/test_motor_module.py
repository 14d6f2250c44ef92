"""The NPMP motor module (learner/motor_module.py): prior, KL, shapes, learning, decoder exports."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from learner.errors import SfvError
from learner.motor_config import MotorModuleConfig
from learner.motor_decoder import LatentDecoder, save_decoder_npz
from learner.motor_module import MotorModule, gaussian_kl, prior_params, prior_sample

SMALL = dict(latent_dim=4, encoder_hidden=(16,), decoder_hidden=(16,), proprio_dim=6, future_dim=5, action_dim=3)


def small_module(**overrides) -> MotorModule:
    return MotorModule(MotorModuleConfig(**(SMALL | overrides)), torch.Generator().manual_seed(0))


def test_prior_keeps_its_marginal_variance_at_sigma_squared():
    alpha, sigma = 0.95, 1.7
    gen = torch.Generator().manual_seed(1)
    z = sigma * torch.randn(20000, 3, generator=gen)  # start at the stationary marginal
    for _ in range(60):
        z = prior_sample(z, alpha, sigma, torch.randn(z.shape, generator=gen))
    assert z.var(dim=0).numpy() == pytest.approx(np.full(3, sigma ** 2), rel=0.05)
    # successive steps correlate by alpha
    nxt = prior_sample(z, alpha, sigma, torch.randn(z.shape, generator=gen))
    corr = ((z * nxt).mean(0) / (z.std(0) * nxt.std(0))).numpy()
    assert corr == pytest.approx(np.full(3, alpha), abs=0.01)
    mean, std = prior_params(z[:2], alpha, sigma, z[:2])
    assert torch.allclose(mean, alpha * z[:2]) and torch.allclose(std, torch.full_like(std, math.sqrt(1 - alpha ** 2) * sigma))
    mean, std = prior_params(None, alpha, sigma, z[:2])
    assert torch.all(mean == 0) and torch.allclose(std, torch.full_like(std, sigma))


def test_kl_matches_a_monte_carlo_estimate():
    gen = torch.Generator().manual_seed(2)
    mu_q, std_q = torch.tensor([0.3, -1.0, 2.0]), torch.tensor([0.5, 1.2, 0.1])
    mu_p, std_p = torch.tensor([0.0, 0.5, 1.5]), torch.tensor([1.0, 0.8, 0.3])
    z = mu_q + std_q * torch.randn(400000, 3, generator=gen, dtype=torch.float64)
    q = torch.distributions.Normal(mu_q.double(), std_q.double())
    p = torch.distributions.Normal(mu_p.double(), std_p.double())
    monte_carlo = (q.log_prob(z) - p.log_prob(z)).mean(0)
    analytic = gaussian_kl(mu_q, std_q, mu_p, std_p)
    assert analytic.numpy() == pytest.approx(monte_carlo.numpy(), abs=0.02)
    assert float(gaussian_kl(mu_q, std_q, mu_q, std_q).abs().max()) < 1e-6


def test_encoder_and_decoder_shapes():
    module = small_module()
    future, z_prev, proprio = torch.randn(7, 5), torch.randn(7, 4), torch.randn(7, 6)
    mu, std = module.encode(future, z_prev)
    assert mu.shape == std.shape == (7, 4) and bool((std > 0).all())
    assert module.decode(proprio, mu).shape == (7, 3)
    terms = module.sequence_loss(torch.randn(2, 4, 6), torch.randn(2, 4, 5), torch.randn(2, 4, 3))
    assert set(terms) == {"loss", "nll", "kl", "rmse"} and all(t.shape == () for t in terms.values())
    with pytest.raises(RuntimeError):
        module.encode(torch.randn(7, 6), z_prev)  # a future of the wrong width


def synthetic_sequences(rng: np.random.Generator, batch: int, window: int):
    """Targets that depend on the future (which only the encoder sees) and on the proprioception."""
    proprio = rng.standard_normal((batch, window, 6)).astype(np.float32)
    future = rng.standard_normal((batch, window, 5)).astype(np.float32)
    targets = np.stack((future[..., 0] + 0.5 * proprio[..., 1], future[..., 1] * future[..., 2], proprio[..., 0]), -1)
    return [torch.from_numpy(a) for a in (proprio, future, targets.astype(np.float32))]


def test_loss_decreases_on_a_tiny_synthetic_dataset():
    torch.manual_seed(0)
    module = small_module(encoder_hidden=(32,), decoder_hidden=(32,), beta=0.01)
    rng = np.random.default_rng(3)
    optimiser = torch.optim.Adam(module.parameters(), lr=3e-3)
    gen = torch.Generator().manual_seed(4)
    held = synthetic_sequences(np.random.default_rng(99), 64, 4)
    with torch.no_grad():
        before = module.sequence_loss(*held, sample=False)
    for _ in range(300):
        loss = module.sequence_loss(*synthetic_sequences(rng, 32, 4), gen)["loss"]
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
    with torch.no_grad():
        after = module.sequence_loss(*held, sample=False)
    assert float(after["loss"]) < float(before["loss"]) - 1.0
    assert float(after["rmse"]) < 0.6 * float(before["rmse"])  # the targets' first column needs the encoder's z


def test_a_fixed_decoder_std_stays_put_while_a_learned_one_moves():
    rng = np.random.default_rng(5)
    for learn in (True, False):
        torch.manual_seed(0)
        module = small_module(encoder_hidden=(32,), decoder_hidden=(32,), learn_action_std=learn, init_action_std=0.3)
        optimiser = torch.optim.Adam(module.parameters(), lr=3e-3)
        gen = torch.Generator().manual_seed(4)
        for _ in range(100):
            loss = module.sequence_loss(*synthetic_sequences(rng, 32, 4), gen)["loss"]
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
        std = module.normalised_action_std().detach()
        assert torch.allclose(std, torch.full_like(std, 0.3)) != learn


def test_numpy_and_onnx_decoders_equal_the_torch_decoder(tmp_path):
    pytest.importorskip("onnxruntime")
    from learner.motor_decoder_onnx import OnnxLatentDecoder, export_decoder_onnx

    module = small_module()
    rng = np.random.default_rng(5)
    module.set_normalisation(rng.normal(2, 3, (50, 6)), rng.normal(0, 1, (50, 5)), rng.normal(0.5, 0.2, (50, 3)))
    with torch.no_grad():
        for p in module.decoder.parameters():
            p.add_(0.3 * torch.randn(p.shape, generator=torch.Generator().manual_seed(6)))
    proprio, z = rng.normal(2, 3, (9, 6)).astype(np.float32), rng.standard_normal((9, 4)).astype(np.float32)
    with torch.no_grad():
        expected = module.decode(torch.from_numpy(proprio), torch.from_numpy(z)).numpy()
    weights = module.decoder_weights()
    save_decoder_npz(weights, tmp_path / "decoder.npz")
    export_decoder_onnx(weights, tmp_path / "decoder.onnx")
    numpy_decoder = LatentDecoder.load(tmp_path)
    assert numpy_decoder(proprio, z) == pytest.approx(expected, abs=1e-5)
    assert OnnxLatentDecoder(tmp_path / "decoder.onnx")(proprio, z) == pytest.approx(expected, abs=1e-5)
    assert numpy_decoder.action_std == pytest.approx(module.action_std().detach().numpy())
    assert np.abs(expected).max() > 0.1  # not a trivially zero output


def test_decoder_files_with_faults_are_one_clear_error(tmp_path):
    weights = small_module().decoder_weights()
    broken = dict(weights)
    broken["layer1.weight"] = broken["layer1.weight"][:5]
    np.savez(tmp_path / "bad.npz", **broken)
    with pytest.raises(SfvError, match="bad.npz.*layer1"):
        LatentDecoder.load(tmp_path / "bad.npz")
    with pytest.raises(SfvError, match="not found"):
        LatentDecoder.load(tmp_path / "missing")
    with pytest.raises(SfvError, match="alpha"):
        MotorModuleConfig(alpha=1.0)
