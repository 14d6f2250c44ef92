"""Observation normaliser statistics and the fixed-std Gaussian policy head."""

import math

import numpy as np
import pytest
import torch

from learner.networks import ObservationNormalizer, PolicyNetwork, ValueNetwork


def test_normalizer_matches_numpy_over_uneven_batches():
    rng = np.random.default_rng(0)
    scales = np.array([0.01, 1.0, 30.0, 1e3])
    blocks = [rng.normal(loc=[5.0, -2.0, 0.0, 1e4], scale=scales, size=(size, 4)) for size in (1, 7, 300, 64, 2)]
    normalizer = ObservationNormalizer(4, clip=10.0, max_samples=10**9)
    for block in blocks:
        normalizer.update(torch.as_tensor(block, dtype=torch.float32))
    everything = np.concatenate([block.astype(np.float32).astype(np.float64) for block in blocks])
    np.testing.assert_allclose(normalizer.mean.numpy(), everything.mean(0), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(normalizer.var.numpy(), everything.var(0), rtol=1e-9)
    assert int(normalizer.count) == len(everything)


def test_normalizer_freezes_after_max_samples():
    normalizer = ObservationNormalizer(2, clip=10.0, max_samples=5)
    normalizer.update(torch.tensor([[0.0, 0.0], [2.0, 4.0], [4.0, 8.0]]))
    normalizer.update(torch.tensor([[6.0, 12.0], [8.0, 16.0], [1000.0, 1000.0]]))  # third row is past the cap
    normalizer.update(torch.tensor([[-500.0, -500.0]]))
    np.testing.assert_allclose(normalizer.mean.numpy(), [4.0, 8.0])
    np.testing.assert_allclose(normalizer.var.numpy(), [8.0, 32.0])
    assert normalizer.frozen


def test_normalized_output_is_standardised_and_clipped():
    normalizer = ObservationNormalizer(1, clip=3.0, max_samples=100)
    normalizer.update(torch.tensor([[1.0], [3.0]]))  # mean 2, std 1
    out = normalizer(torch.tensor([[2.5], [100.0], [-100.0]]))
    np.testing.assert_allclose(out.numpy().ravel(), [0.5, 3.0, -3.0], rtol=1e-6)


def test_policy_log_prob_is_fixed_std_gaussian():
    policy = PolicyNetwork(5, 3, (16, 8), action_std=0.2, generator=torch.Generator().manual_seed(1))
    obs = torch.randn(4, 5, generator=torch.Generator().manual_seed(2))
    actions = torch.randn(4, 3, generator=torch.Generator().manual_seed(3))
    mean = policy(obs).detach()
    by_hand = (-0.5 * ((actions - mean) / 0.2) ** 2 - math.log(0.2) - 0.5 * math.log(2 * math.pi)).sum(-1)
    torch.testing.assert_close(policy.log_prob(obs, actions).detach(), by_hand, rtol=1e-5, atol=1e-5)
    # The std is a buffer: saved with the weights, never handed to an optimiser.
    assert "log_std" in policy.state_dict()
    assert not policy.log_std.requires_grad
    assert not any(parameter is policy.log_std for parameter in policy.parameters())
    assert len(list(policy.parameters())) == 6  # three Linear layers


def test_init_is_reproducible_and_policy_mean_starts_near_zero():
    def build(seed):
        generator = torch.Generator().manual_seed(seed)
        return PolicyNetwork(10, 4, (64, 32), 0.1, generator), ValueNetwork(10, (64, 32), generator)

    (policy_a, value_a), (policy_b, _value_b), (policy_c, _) = build(7), build(7), build(8)
    for left, right in zip(list(policy_a.state_dict().values()), list(policy_b.state_dict().values())):
        assert torch.equal(left, right)
    assert not torch.equal(policy_a.mean_net[0].weight, policy_c.mean_net[0].weight)
    obs = torch.randn(256, 10)
    assert policy_a(obs).abs().max() < 0.1  # small output gain: the neutral action
    assert value_a(obs).shape == (256,)


@pytest.mark.parametrize("bad", [0.0, -1.0])
def test_config_rejects_non_positive_std(bad):
    from learner.config import PPOConfig
    from learner.errors import SfvError

    with pytest.raises(SfvError, match="action_std"):
        PPOConfig(action_std=bad)


def test_a_bfloat16_value_network_regresses_like_the_float32_one():
    """The same init, the same 200 Adam steps on a smooth target: the bfloat16 network's values stay
    float32, differ from float32 arithmetic (the flag is in force) and fit as well to within 10 %."""
    rng = np.random.default_rng(0)
    x = torch.as_tensor(rng.normal(size=(512, 32)), dtype=torch.float32)
    y = torch.sin(x[:, 0]) + 0.5 * x[:, 1] ** 2
    losses, outputs = {}, {}
    for bf16 in (False, True):
        net = ValueNetwork(32, (128, 64), torch.Generator().manual_seed(3), bfloat16=bf16)
        optimizer = torch.optim.Adam(net.parameters(), lr=1e-3)
        for _ in range(200):
            loss = (net(x) - y).square().mean()
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
        with torch.no_grad():
            outputs[bf16] = net(x)
            losses[bf16] = float((outputs[bf16] - y).square().mean())
    assert outputs[True].dtype == torch.float32
    assert not torch.equal(outputs[True], outputs[False])
    assert losses[True] < 1.1 * losses[False] + 1e-3
    assert losses[False] < 0.1 * float(y.var())  # both actually learnt the target
