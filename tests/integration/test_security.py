"""Refusing bad requests end to end: ASI token and TLS, Redis password, checkpoint integrity.

Real `sfv asi-server` subprocesses and redis-server; training runs through the `sfv train`
entry point (a subprocess where the process boundary matters, services.cli.main otherwise).
"""
from __future__ import annotations

import datetime
import io
import ipaddress
import shutil
import subprocess
import sys

import pytest
import torch

from actors.rollout.asi_client import ASIClient
from learner.checkpoint import load_checkpoint
from learner.errors import SfvError
from services.cli import main
from services.training.config import TrainConfig
from services.training.driver import Trainer
from services.training.run_dir import checkpoint_files, read_metrics, run_checkpoint
from tests.asi_helpers import ServerProcess
from tests.redis_fixture import redis_server_with_password  # noqa: F401  (fixture)
from tests.integration.test_faults_support import REPO, TINY_RUN, TrainProcess, clean_env

pytestmark = pytest.mark.integration

TOKEN = "tok-5f1c0e9a7b3d4c21"
ONE_ITERATION = ("--serial", "--workers", "1", "--envs-per-worker", "4", "--init", "asi", "--samples", "256", *TINY_RUN)


def last_error_line(capsys) -> str:
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines, "no error message"
    return lines[-1]


# ---------------------------------------------------------------------------------- ASI token
def test_asi_token_required_end_to_end(tmp_path, monkeypatch, capsys):
    server = ServerProcess(tmp_path / "asi.log", "--port", "0", env={"SFV_ASI_TOKEN": TOKEN})
    address = server.wait_listening()
    try:
        with TrainProcess(tmp_path / "ok", *ONE_ITERATION, "--asi-address", address,
                          env=clean_env(SFV_ASI_TOKEN=TOKEN)) as train:
            assert train.wait(300) == 0, train.output()
        assert read_metrics(train.out)[-1]["samples"] == 256

        for label, token in (("no token", None), ("wrong token", TOKEN + "x")):
            if token is None:
                monkeypatch.delenv("SFV_ASI_TOKEN", raising=False)
            else:
                monkeypatch.setenv("SFV_ASI_TOKEN", token)
            code = main(["train", *ONE_ITERATION, "--asi-address", address, "--out", str(tmp_path / label.replace(" ", "-"))])
            message = last_error_line(capsys)
            assert code == 2, label
            assert message.startswith(f"sfv: asi server {address}: create job") and "UNAUTHENTICATED" in message, message
            assert TOKEN not in message
    finally:
        assert server.stop() == 0
    assert TOKEN not in server.log_text() and TOKEN not in train.stderr() and TOKEN not in train.stdout()


# ---------------------------------------------------------------------------------------- TLS
def self_signed(directory, name: str) -> tuple[str, str]:
    """(cert.pem, key.pem) for 127.0.0.1 / localhost, made with `cryptography` or the openssl CLI."""
    cert_path, key_path = directory / f"{name}.crt", directory / f"{name}.key"
    try:
        from cryptography import x509
        from cryptography.hazmat.primitives import hashes, serialization
        from cryptography.hazmat.primitives.asymmetric import ec
        from cryptography.x509.oid import NameOID
    except ImportError:
        if shutil.which("openssl") is None:
            pytest.skip("neither the cryptography package nor the openssl CLI is available")
        subprocess.run(["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
                        "-keyout", str(key_path), "-out", str(cert_path), "-days", "1", "-subj", "/CN=localhost",
                        "-addext", "subjectAltName=IP:127.0.0.1,DNS:localhost"], check=True, capture_output=True)
        return str(cert_path), str(key_path)
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "localhost")])
    now = datetime.datetime.now(datetime.timezone.utc)
    cert = (x509.CertificateBuilder().subject_name(subject).issuer_name(subject).public_key(key.public_key())
            .serial_number(x509.random_serial_number()).not_valid_before(now - datetime.timedelta(hours=1))
            .not_valid_after(now + datetime.timedelta(days=1))
            .add_extension(x509.SubjectAlternativeName([x509.DNSName("localhost"),
                                                        x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]), critical=False)
            .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
            .sign(key, hashes.SHA256()))
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_path.write_bytes(key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                           serialization.NoEncryption()))
    return str(cert_path), str(key_path)


def test_asi_tls_end_to_end(tmp_path, capsys):
    cert, key = self_signed(tmp_path, "server")
    other_ca, _ = self_signed(tmp_path, "other")
    server = ServerProcess(tmp_path / "asi.log", "--port", "0", "--tls-cert", cert, "--tls-key", key)
    address = server.wait_listening()
    try:
        code = main(["train", *ONE_ITERATION, "--asi-address", address, "--asi-tls-ca", cert, "--out", str(tmp_path / "tls")])
        assert code == 0, capsys.readouterr().err
        assert read_metrics(tmp_path / "tls")[-1]["samples"] == 256
        # A plaintext client, or one that trusts another CA, never gets a channel to the TLS server.
        for label, ca in (("plaintext", None), ("untrusted CA", other_ca)):
            with ASIClient(address, "probe", tls_root_cert=ca) as client:
                with pytest.raises(SfvError, match="not reachable"):
                    client.wait_until_ready(timeout=2.0)
        code = main(["train", *ONE_ITERATION, "--asi-address", address, "--asi-tls-ca", str(tmp_path / "missing.pem"),
                     "--out", str(tmp_path / "no-ca")])
        assert code == 2 and "missing.pem: cannot read TLS root certificate" in last_error_line(capsys)
        code = main(["train", *ONE_ITERATION, "--asi-tls-ca", cert, "--out", str(tmp_path / "embedded")])
        assert code == 2 and "--asi-tls-ca needs --asi-address" in last_error_line(capsys)
    finally:
        assert server.stop() == 0


# --------------------------------------------------------------------------------- Redis auth
def test_redis_password_honoured_and_never_printed(tmp_path, redis_server_with_password, capsys):  # noqa: F811
    import redis

    server = redis_server_with_password
    code = main(["train", *ONE_ITERATION, "--redis-url", server.url, "--out", str(tmp_path / "ok")])
    assert code == 0, capsys.readouterr().err
    client = redis.Redis(host="127.0.0.1", port=server.port, password=server.password)
    try:
        assert client.keys("*"), "the ASI job was not stored in the password-protected Redis"
    finally:
        client.close()
    wrong = "not-the-pw-93c1"
    for label, url in (("wrong password", server.url.replace(server.password, wrong)),
                       ("no password", f"redis://127.0.0.1:{server.port}/0")):
        code = main(["train", *ONE_ITERATION, "--redis-url", url, "--out", str(tmp_path / label.replace(" ", "-"))])
        message = last_error_line(capsys)
        assert code == 2 and message.startswith("sfv: redis at redis://") and "unreachable" in message, (label, message)
        assert wrong not in message and server.password not in message, message


# -------------------------------------------------------------------------------- checkpoints
@pytest.fixture(scope="module")
def trained_run(tmp_path_factory):
    """A finished 2-iteration run (two checkpoints), trained once for the checkpoint tests."""
    out = tmp_path_factory.mktemp("trained") / "run"
    config = TrainConfig(out=str(out), workers=1, envs_per_worker=4, init="rsi", samples=512, runner="in_process",
                         checkpoint_every=1, plot_every=0)
    config.ppo.batch_size, config.ppo.minibatch_size = 256, 128
    config.ppo.policy_hidden = config.ppo.value_hidden = (64, 32)
    Trainer(config, progress=False).run()
    return out


def test_checkpoints_load_with_weights_only(trained_run):
    newest = checkpoint_files(trained_run)[-1]
    envelope = torch.load(newest, map_location="cpu", weights_only=True)
    payload = torch.load(io.BytesIO(envelope["payload"].numpy().tobytes()), map_location="cpu", weights_only=True)
    assert payload["samples"] == 512 and set(payload) >= {"learner", "policy_weights", "iteration", "config"}


class _RunsCode:
    """Pickles into a call of `exec`; a loader that unpickles arbitrary objects would run it."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (exec, (f"open({str(self.marker)!r}, 'w').close()",))


def tamper(path, how: str, marker) -> None:
    data = bytearray(path.read_bytes())
    if how == "flipped byte":
        data[len(data) // 2] ^= 0x40  # inside the payload's bytes, which fill most of the file
        path.write_bytes(bytes(data))
    elif how == "truncated":
        path.write_bytes(bytes(data[: len(data) // 3]))
    else:  # a pickle that runs code when loaded without weights_only
        torch.save({"format": "sfv-checkpoint", "version": 1, "payload": _RunsCode(marker)}, path)


@pytest.mark.parametrize("how", ["flipped byte", "truncated", "code-running pickle"])
def test_eval_refuses_a_tampered_checkpoint_it_reads(how, trained_run, tmp_path, capsys):
    run = tmp_path / "run"
    shutil.copytree(trained_run, run)
    newest = run_checkpoint(run)  # best.pt: the run was evaluated at its end
    assert newest.name == "best.pt" and checkpoint_files(run)
    marker = tmp_path / "code-ran"
    tamper(newest, how, marker)
    if how == "flipped byte":  # the real command line, once
        done = subprocess.run([sys.executable, "-m", "services.cli", "eval", str(run), "--episodes", "1"], cwd=REPO,
                              env=clean_env(), capture_output=True, text=True, timeout=300)
        code, message = done.returncode, done.stderr.strip().splitlines()[-1]
    else:
        code = main(["eval", str(run), "--episodes", "1"])
        message = last_error_line(capsys)
    assert code == 2
    assert message.startswith(f"sfv: {newest}: checkpoint is truncated or corrupt"), message
    if how == "flipped byte":
        assert "SHA-256" in message, message
    assert not marker.exists(), "loading the checkpoint ran code"
    assert load_checkpoint(checkpoint_files(run)[0])["samples"] == 256  # the older one is intact, yet not used silently
