"""ASI stores: batching of reports into gradient steps, atomicity, Redis persistence and failures."""
import socket
import threading
import time

import numpy as np
import pytest

from learner.errors import SfvError
from services.asi.distribution import InitialStateDistribution, UpdateConfig, evenly_spaced_phases
from services.asi.fall_weights import FallStats
from services.asi.store import EpisodeBatch, InMemoryStore, JobSpec
from tests.redis_fixture import redis_server_with_password  # noqa: F401  (fixture)

K, D, FRAMES = 3, 4, 12


def make_spec(job_id="job", episodes_per_update=10, fall_weighting=0.0) -> tuple[JobSpec, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    reference = rng.normal(size=(FRAMES, D)).astype(np.float32)
    ref_phases = np.linspace(0, 1, FRAMES)
    config = UpdateConfig(step_size=0.05, episodes_per_update=episodes_per_update, max_step_fraction=0.0,
                          fall_weighting=fall_weighting)
    dist = InitialStateDistribution.from_reference(reference, ref_phases, K)
    return JobSpec(job_id, config, evenly_spaced_phases(K), reference, ref_phases), dist.means, dist.log_stds


def make_batch(n, seed) -> EpisodeBatch:
    rng = np.random.default_rng(seed)
    return EpisodeBatch(rng.normal(size=(n, D)).astype(np.float32), rng.integers(K, size=n).astype(np.int32),
                        rng.normal(size=n))


def expected_after(spec, means, log_stds, batches):
    """Replay: one numpy step per full batch of episodes_per_update, in report order."""
    allbatch = EpisodeBatch.concatenate(batches)
    per = spec.config.episodes_per_update
    dist = InitialStateDistribution(spec.phases, means, log_stds)
    steps = len(allbatch) // per
    for i in range(steps):
        used = allbatch.split((i + 1) * per)[0].split(i * per)[1]
        dist = dist.apply_update(used.states, used.components, used.returns, spec.config)
    return dist, steps, len(allbatch) - steps * per


@pytest.fixture(params=["memory", pytest.param("redis", marks=pytest.mark.integration)])
def store(request):
    if request.param == "memory":
        yield InMemoryStore()
    else:
        from services.asi.redis_store import RedisStore

        store = RedisStore(request.getfixturevalue("redis_url"))
        yield store
        store.close()


def test_episode_batch_bytes_round_trip():
    batch = make_batch(7, 1)
    back = EpisodeBatch.from_bytes(batch.to_bytes())
    np.testing.assert_array_equal(back.states, batch.states)
    np.testing.assert_array_equal(back.components, batch.components)
    np.testing.assert_array_equal(back.returns, batch.returns)


def test_create_is_idempotent(store):
    spec, means, log_stds = make_spec()
    _, params, created = store.create_job(spec, means, log_stds)
    assert created and params.version == 0
    store.report(spec, make_batch(12, 0), None)
    other_means = means + 1.0
    stored, params, created = store.create_job(spec, other_means, log_stds)
    assert not created
    assert params.version == 1 and params.pending_episodes == 2
    np.testing.assert_array_equal(stored.reference_states, spec.reference_states)
    assert not np.array_equal(params.means, other_means)  # the existing parameters win


def test_reports_step_once_per_full_batch_and_match_numpy(store):
    spec, means, log_stds = make_spec(episodes_per_update=10)
    store.create_job(spec, means, log_stds)
    batches = [make_batch(n, seed) for seed, n in enumerate([4, 5, 3, 17, 1, 9])]  # 39 episodes
    outcomes = [store.report(spec, b, policy_version=seed) for seed, b in enumerate(batches)]
    assert [o.version for o in outcomes] == [0, 0, 1, 2, 3, 3]  # cumulative 4, 9, 12, 29, 30, 39
    assert [o.updated for o in outcomes] == [False, False, True, True, True, False]
    expected, steps, pending = expected_after(spec, means, log_stds, batches)
    params = store.get_params(spec.job_id)
    assert (params.version, params.pending_episodes, params.policy_version) == (steps, pending, 5)
    np.testing.assert_array_equal(params.means, expected.means)
    np.testing.assert_array_equal(params.log_stds, expected.log_stds)


def test_concurrent_reports_never_lose_or_reuse_episodes(store):
    spec, means, log_stds = make_spec(episodes_per_update=25)
    store.create_job(spec, means, log_stds)
    threads = [threading.Thread(target=lambda s=s: [store.report(spec, make_batch(3, s * 100 + i), None)
                                                    for i in range(20)]) for s in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    params = store.get_params(spec.job_id)
    assert (params.version, params.pending_episodes) == divmod(4 * 20 * 3, 25)


def test_unknown_job_is_none(store):
    assert store.get_spec("nope") is None and store.get_params("nope") is None


def fall_flags(batch: EpisodeBatch) -> np.ndarray:
    """Component 2 always falls, the others never."""
    return batch.components == 2


def test_fall_flags_feed_the_rates_and_a_report_without_them_leaves_them(store):
    spec, means, log_stds = make_spec(fall_weighting=0.5)
    store.create_job(spec, means, log_stds)
    store.report(spec, make_batch(12, 0), None)  # an old client: no flags
    assert store.get_params(spec.job_id).fall_stats is None
    np.testing.assert_array_equal(store.get_params(spec.job_id).fall_rates(), np.zeros(K))
    flagged = [make_batch(n, seed) for seed, n in ((1, 7), (2, 9))]
    expected = FallStats.empty(K)
    for batch in flagged:
        store.report(spec, batch, None, fall_flags(batch))
        expected = expected.updated(batch.components, fall_flags(batch))
        store.report(spec, make_batch(3, 9), None)  # unflagged reports in between change nothing
    np.testing.assert_array_equal(store.get_params(spec.job_id).fall_rates(), [0.0, 0.0, 1.0])
    _, resumed, created = store.create_job(spec, means, log_stds)  # a resumed run re-creates its job
    assert not created
    np.testing.assert_array_equal(resumed.fall_stats.falls, expected.falls)
    np.testing.assert_array_equal(resumed.fall_stats.episodes, expected.episodes)


def test_concurrent_flagged_reports_never_lose_a_flag(store):
    spec, means, log_stds = make_spec(episodes_per_update=25)
    store.create_job(spec, means, log_stds)
    batch = EpisodeBatch(np.zeros((3, D), np.float32), np.zeros(3, np.int32), np.zeros(3))
    fell = np.array([True, False, True])
    threads = [threading.Thread(target=lambda: [store.report(spec, batch, None, fell) for _ in range(20)]) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    expected = FallStats.empty(K)
    for _ in range(80):  # identical reports: the result does not depend on their order, only on none being lost
        expected = expected.updated(batch.components, fell)
    stats = store.get_params(spec.job_id).fall_stats
    np.testing.assert_allclose(stats.episodes, expected.episodes, rtol=1e-12)
    np.testing.assert_allclose(stats.falls, expected.falls, rtol=1e-12)


@pytest.mark.integration
def test_redis_and_memory_stores_agree_on_fall_stats_and_weighted_steps(redis_url):
    from services.asi.redis_store import RedisStore

    spec, means, log_stds = make_spec(episodes_per_update=10, fall_weighting=0.5)
    memory, redis_store = InMemoryStore(), RedisStore(redis_url)
    batches = [make_batch(n, seed) for seed, n in enumerate([4, 8, 13, 2])]
    for store in (memory, redis_store):
        store.create_job(spec, means, log_stds)
        for batch in batches:
            store.report(spec, batch, None, fall_flags(batch))
    again = RedisStore(redis_url)  # a restarted server's store object
    assert again.get_spec(spec.job_id).config == spec.config  # fall_weighting kept with the job
    a, b = memory.get_params(spec.job_id), again.get_params(spec.job_id)
    assert a.version == b.version == 2
    np.testing.assert_array_equal(a.fall_stats.falls, b.fall_stats.falls)
    np.testing.assert_array_equal(a.fall_stats.episodes, b.fall_stats.episodes)
    np.testing.assert_array_equal(a.means, b.means)
    np.testing.assert_array_equal(a.log_stds, b.log_stds)
    redis_store.close()
    again.close()


@pytest.mark.integration
def test_redis_store_survives_a_new_store_object_and_a_redis_restart(redis_server):
    from services.asi.redis_store import RedisStore

    spec, means, log_stds = make_spec()
    first = RedisStore(redis_server.url)
    first.create_job(spec, means, log_stds)
    first.report(spec, make_batch(23, 5), None)
    before = first.get_params(spec.job_id)
    first.close()
    redis_server.restart()  # same port, data kept through an RDB dump
    second = RedisStore(redis_server.url)
    after = second.get_params(spec.job_id)
    assert (after.version, after.pending_episodes) == (before.version, before.pending_episodes) == (2, 3)
    np.testing.assert_array_equal(after.means, before.means)
    np.testing.assert_array_equal(after.log_stds, before.log_stds)
    stored = second.get_spec(spec.job_id)
    np.testing.assert_array_equal(stored.reference_states, spec.reference_states)
    assert stored.config == spec.config
    assert second.report(spec, make_batch(7, 6), None).version == 3  # the 3 pending ones count
    second.close()


@pytest.mark.integration
def test_redis_unreachable_fails_fast_with_redacted_url():
    from services.asi.redis_store import RedisStore

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]  # nothing listens here
    start = time.monotonic()
    with pytest.raises(SfvError) as err:
        RedisStore(f"redis://:hunter2@127.0.0.1:{port}/0")
    assert time.monotonic() - start < 5
    assert f"127.0.0.1:{port}" in str(err.value) and "hunter2" not in str(err.value) and "***" in str(err.value)


@pytest.mark.integration
def test_redis_that_never_answers_times_out_instead_of_hanging():
    from services.asi.redis_store import RedisStore

    with socket.socket() as silent:  # accepts TCP connections (backlog) but never replies
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        start = time.monotonic()
        with pytest.raises(SfvError, match="unreachable"):
            RedisStore(f"redis://127.0.0.1:{silent.getsockname()[1]}/0", connect_timeout=0.5)
        assert time.monotonic() - start < 5


@pytest.mark.integration
def test_redis_password_is_honoured_and_never_shown(redis_server_with_password):  # noqa: F811
    from services.asi.redis_store import RedisStore

    good = RedisStore(redis_server_with_password.url)
    spec, means, log_stds = make_spec()
    assert good.create_job(spec, means, log_stds)[2]
    good.close()
    wrong = redis_server_with_password.url.replace(redis_server_with_password.password, "wrong-pw")
    with pytest.raises(SfvError) as err:
        RedisStore(wrong)
    assert "wrong-pw" not in str(err.value) and "***" in str(err.value)
    with pytest.raises(SfvError):
        RedisStore(redis_server_with_password.url.replace(f":{redis_server_with_password.password}@", ""))
