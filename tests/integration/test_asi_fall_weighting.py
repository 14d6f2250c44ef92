"""Failure-weighted ASI components end to end: real gRPC server and client (and real Redis where named)."""
import grpc
import numpy as np
import pytest

from actors.rollout.asi_client import ASIClient
from learner.errors import SfvError
from proto import asi_pb2_grpc
from services.asi.distribution import InitialStateDistribution
from services.asi.server import serve
from services.asi.store import InMemoryStore
from tests.asi_helpers import D, create_request, reference_clip

pytestmark = pytest.mark.integration
K = 10
FALLING = 3


@pytest.fixture
def server():
    running, _ = serve(0, InMemoryStore())
    yield running
    running.stop(None).wait()


def new_job(address: str, job_id: str, beta: float | None, **settings) -> ASIClient:
    states, phases = reference_clip()
    client = ASIClient(address, job_id)
    client.create_job(states, phases, num_components=K, fall_weighting=beta, **settings)
    return client


def report_falls(client: ASIClient, flags: bool = True) -> None:
    """200 episodes, 20 per component: component 3's all fell, the others' none."""
    components = np.repeat(np.arange(K), 20).astype(np.int32)
    states = np.zeros((components.size, D), np.float32)
    client.report(states, components, np.zeros(components.size), fell=components == FALLING if flags else None)


def drawn_share(client: ASIClient, draws: int = 4 * 8192) -> np.ndarray:
    counts = np.zeros(K)
    for seed in range(draws // 8192):
        counts += np.bincount(client.sample("asi", 8192, seed=seed).components, minlength=K)
    return counts / draws


def test_an_always_falling_component_is_drawn_at_the_floor_plus_beta(server):
    """beta .5, k 10: component 3 at .05 + .5 = .55 of 32768 seeded draws. Binomial std
    sqrt(.55 * .45 / 32768) = .0027; 4 stds (.011) separate it from every wrong rule:
    uniform .1, no floor .5, no beta 1.0."""
    client = new_job(server.address, "flip", 0.5)
    report_falls(client)
    dist = client.get_distribution()
    np.testing.assert_array_equal(dist.fall_rates, np.eye(K)[FALLING])
    np.testing.assert_allclose(dist.weights, 0.05 + 0.5 * np.eye(K)[FALLING], rtol=1e-12)
    share = drawn_share(client)
    assert abs(share[FALLING] - 0.55) < 4 * np.sqrt(0.55 * 0.45 / 32768)
    assert np.all(np.abs(np.delete(share, FALLING) - 0.05) < 4 * np.sqrt(0.05 * 0.95 / 32768))
    client.close()


def test_beta_zero_draws_exactly_the_papers_uniform_components(server):
    client = new_job(server.address, "paper", None)
    report_falls(client)
    dist = client.get_distribution()
    np.testing.assert_array_equal(dist.weights, np.full(K, 0.1))
    np.testing.assert_array_equal(dist.fall_rates, np.eye(K)[FALLING])  # measured all the same
    draw = client.sample("asi", 500, seed=4)
    expected = InitialStateDistribution(dist.phases, dist.means, np.log(dist.stds)).sample(np.random.default_rng(4), 500)
    np.testing.assert_array_equal(draw.components, expected[1])
    np.testing.assert_array_equal(draw.states, expected[0])
    client.close()


def test_reports_without_fall_flags_leave_the_weights_uniform(server):
    client = new_job(server.address, "old-client", 0.9)
    report_falls(client, flags=False)
    dist = client.get_distribution()
    np.testing.assert_array_equal(dist.weights, np.full(K, 0.1))
    np.testing.assert_array_equal(dist.fall_rates, np.zeros(K))
    client.close()


@pytest.mark.parametrize("beta", [-0.1, 1.5, float("nan"), float("inf")])
def test_a_bad_beta_is_refused_in_one_line(server, beta):
    with grpc.insecure_channel(server.address) as channel:
        with pytest.raises(grpc.RpcError) as err:
            asi_pb2_grpc.InitialStateServiceStub(channel).CreateJob(create_request("bad", fall_weighting=beta), timeout=5)
    assert err.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    assert "fall_weighting" in err.value.details() and "\n" not in err.value.details()
    with pytest.raises(SfvError, match="INVALID_ARGUMENT: fall_weighting"):
        new_job(server.address, "bad-client", beta)


def test_the_weights_survive_a_resumed_job_on_the_same_server(server):
    client = new_job(server.address, "resume", 0.5)
    report_falls(client)
    before = client.get_distribution()
    client.close()
    again = new_job(server.address, "resume", 0.5)  # what a resumed run's driver does
    after = again.get_distribution()
    np.testing.assert_array_equal(after.weights, before.weights)
    np.testing.assert_array_equal(after.fall_rates, before.fall_rates)
    again.close()


def test_redis_and_memory_servers_agree_and_redis_keeps_the_weights_across_a_restart(redis_url, server):
    from services.asi.redis_store import RedisStore

    running, _ = serve(0, RedisStore(redis_url))
    on_redis, in_memory = new_job(running.address, "agree", 0.5), new_job(server.address, "agree", 0.5)
    for client in (on_redis, in_memory):
        report_falls(client)
    before = on_redis.get_distribution()
    np.testing.assert_array_equal(before.weights, in_memory.get_distribution().weights)
    np.testing.assert_array_equal(on_redis.sample("asi", 300, seed=2).components,
                                  in_memory.sample("asi", 300, seed=2).components)
    on_redis.close()
    running.stop(None).wait()
    restarted, _ = serve(0, RedisStore(redis_url))
    try:
        resumed = new_job(restarted.address, "agree", 0.5)
        after = resumed.get_distribution()
        np.testing.assert_array_equal(after.weights, before.weights)
        np.testing.assert_array_equal(after.fall_rates, before.fall_rates)
        resumed.close()
    finally:
        restarted.stop(None).wait()
    in_memory.close()


def test_a_rollout_worker_reports_each_episodes_fall_flag(walk_clip):
    """A real worker (MuJoCo env, gRPC client): the server's fall statistics are exactly those
    of the episodes the worker's batch lists, so the flags arrive, one per episode, in order."""
    from actors.character.features import observation_dim
    from actors.envs.imitation_env import EnvConfig
    from actors.rollout.worker import RolloutWorker, WorkerSpec
    from learner.config import PPOConfig
    from learner.ppo import PPOLearner
    from services.asi.fall_weights import FallStats
    from services.asi.server import EmbeddedASIServer
    from services.training.config import TrainConfig
    from services.training.driver import Trainer

    _, states, phases = Trainer(TrainConfig(out="unused"))._reference_table(walk_clip)
    with EmbeddedASIServer() as embedded:
        with ASIClient(embedded.address, "walk") as client:
            client.create_job(states, phases, num_components=4, fall_weighting=0.5)
            spec = WorkerSpec(walk_clip, EnvConfig(), num_envs=8, init="asi", seed=3, asi_address=embedded.address,
                              asi_job="walk", start_batch=8)
            worker = RolloutWorker(spec)
            obs_dim = observation_dim(len(EnvConfig().reference_obs_steps))
            learner = PPOLearner(obs_dim, worker.action_dim, PPOConfig(policy_hidden=(32,), value_hidden=(32,)))
            batch = worker.sample(learner.policy_weights(), 0, 90)  # 3 s: an untrained walk falls within ~1.1 s
            worker.client.close()
            fell, components = batch["episode_fell"], batch["episode_components"]
            assert fell.any() and len(fell) == len(components)
            expected = FallStats.empty(4).updated(components, fell).rates
            np.testing.assert_allclose(client.get_distribution().fall_rates, expected, rtol=1e-12)
