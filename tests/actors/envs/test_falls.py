"""What counts as a fall (actors/envs/falls.py): DeepMimic's rule, every link but the feet on the
ground ends the episode, with per-clip allowances, and that step earns nothing.

Poses are built here and lowered onto the floor until MuJoCo reports a contact, and the test
checks which geoms touch before asking the detector, so each case is what its name says.
"""
import mujoco
import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.envs.falls import MIN_ROOT_HEIGHT, FallDetector, allowed_contact_links, fall_contact_links
from actors.envs.ground_facts import track_ground_facts
from actors.envs.modes.sfv.config import SfvConfig
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.character.skeleton import JOINT_NAMES, LINK_NAMES
from tests.conftest import load_clip

X, Y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
FEET = {"right_ankle", "left_ankle"}


@pytest.fixture(scope="module")
def humanoid(shared_humanoid):
    return shared_humanoid


@pytest.fixture(scope="module")
def facts(humanoid):
    """Each clip's ground facts, measured on its reference (what its fall rule reads)."""
    names = ("walk", "cartwheel", "backflip", "crawl", "roll", "getup_facedown", "getup_faceup")
    return {name: track_ground_facts(humanoid, ImitationEnv(load_clip(name), EnvConfig(), humanoid).track) for name in names}


@pytest.fixture(scope="module")
def clips():
    return {name: load_clip(name) for name in ("walk", "cartwheel", "roll")}


def qpos_index(humanoid, joint):
    return humanoid.joint_qpos_adr[JOINT_NAMES.index(joint)]


def on_the_floor(humanoid, pose, depth=0.005):
    """MjData with `pose(qpos)` applied, lowered from 3 m until something touches the floor,
    then `depth` further."""
    model = humanoid.model
    data = mujoco.MjData(model)
    pose(data.qpos)
    data.qpos[2] = 3.0
    mujoco.mj_forward(model, data)
    while data.ncon == 0:
        data.qpos[2] -= 0.002
        mujoco.mj_forward(model, data)
    data.qpos[2] -= depth
    mujoco.mj_forward(model, data)
    return data


def touching(humanoid, data) -> set[str]:
    """Links whose geoms are in contact (with the floor: the only pairs there are)."""
    geom_body = humanoid.model.geom_bodyid
    bodies = {int(geom_body[g]) for g in data.contact.geom[: data.ncon].ravel() if g != humanoid.floor_geom_id}
    return {LINK_NAMES[list(humanoid.body_ids).index(b)] for b in bodies}


def kneeling(humanoid):
    """Thighs down, shins flat on the floor behind, feet stretched back."""
    def pose(qpos):
        for side in ("right", "left"):
            qpos[qpos_index(humanoid, f"{side}_knee")] = -np.pi / 2
            a = qpos_index(humanoid, f"{side}_ankle")
            qpos[a:a + 4] = qn.quat_about_axis(-np.pi / 2, Y)
    return pose


def handstand(humanoid):
    """Upside down with both arms overhead: the hands carry the body."""
    def pose(qpos):
        qpos[3:7] = qn.quat_about_axis(np.pi, X)
        for side in ("right", "left"):
            s = qpos_index(humanoid, f"{side}_shoulder")
            qpos[s:s + 4] = qn.quat_about_axis(np.pi, Y)
    return pose


def head_down(humanoid):
    def pose(qpos):
        qpos[3:7] = qn.quat_about_axis(np.pi, X)
    return pose


# ------------------------------------------------------------------ the detector
def test_standing_on_the_feet_is_no_fall(humanoid, facts):
    data = on_the_floor(humanoid, lambda qpos: None)
    assert touching(humanoid, data) == FEET
    for clip in ("walk", "cartwheel", "backflip"):
        assert not FallDetector.for_facts(humanoid, facts[clip])(data)


def test_kneeling_is_a_fall_for_walk(humanoid, facts):
    data = on_the_floor(humanoid, kneeling(humanoid))
    assert touching(humanoid, data) == FEET | {"right_knee", "left_knee"}  # the shins (knee links) lie on the floor
    assert FallDetector.for_facts(humanoid, facts["walk"])(data)
    assert FallDetector.for_facts(humanoid, facts["cartwheel"])(data)  # hands only, not knees
    # Allowing the knees makes it a legal contact; the feet need not be listed.
    assert not FallDetector.for_facts(humanoid, facts["walk"], ("right_knee", "left_knee"))(data)
    assert FallDetector.for_facts(humanoid, facts["walk"], ("right_knee",))(data)


def test_a_hand_on_the_floor_is_no_fall_for_cartwheel_but_is_for_walk(humanoid, facts):
    data = on_the_floor(humanoid, handstand(humanoid))
    assert touching(humanoid, data) == {"right_wrist", "left_wrist"}
    assert not FallDetector.for_facts(humanoid, facts["cartwheel"])(data)
    assert FallDetector.for_facts(humanoid, facts["walk"])(data)
    # An override replaces the clip's allowance: () is feet only, even for the cartwheel.
    assert FallDetector.for_facts(humanoid, facts["cartwheel"], ())(data)


def test_the_head_down_is_a_fall_except_for_clips_on_the_ground(humanoid, facts):
    data = on_the_floor(humanoid, head_down(humanoid))
    assert "neck" in touching(humanoid, data)
    for clip in ("walk", "cartwheel", "crawl"):
        assert FallDetector.for_facts(humanoid, facts[clip])(data), clip
    for clip in ("roll", "getup_facedown", "getup_faceup"):
        assert not FallDetector.for_facts(humanoid, facts[clip])(data), clip
        assert fall_contact_links(facts[clip]).size == 0
    # An explicit override gives a no-rule clip a rule.
    assert FallDetector.for_facts(humanoid, facts["roll"], ())(data)


def test_allowed_links_per_clip(facts):
    assert set(allowed_contact_links(facts["walk"])) == FEET
    assert set(allowed_contact_links(facts["backflip"])) == FEET
    assert set(allowed_contact_links(facts["cartwheel"])) == FEET | {"right_wrist", "left_wrist"}
    assert set(allowed_contact_links(facts["crawl"])) == set(LINK_NAMES) - {"root", "chest", "neck"}
    assert set(allowed_contact_links(facts["roll"])) == set(LINK_NAMES)
    # The fall links are the rest, as skeleton indices.
    assert [LINK_NAMES[i] for i in fall_contact_links(facts["walk"])] == [n for n in LINK_NAMES if n not in FEET]


def test_an_unknown_link_name_is_an_error(facts):
    with pytest.raises(ValueError, match="right_hand"):
        allowed_contact_links(facts["walk"], ("right_hand",))
    with pytest.raises(ValueError, match="tail"):
        fall_contact_links(facts["cartwheel"], ("left_wrist", "tail"))


def test_strict_detector_adds_a_root_height_floor(humanoid, facts):
    data = mujoco.MjData(humanoid.model)  # no contacts computed: only the height can tell
    data.qpos[2] = 0.25
    assert data.ncon == 0
    assert FallDetector.for_facts(humanoid, facts["walk"], strict=True)(data)
    assert not FallDetector.for_facts(humanoid, facts["walk"])(data)
    assert not FallDetector.for_facts(humanoid, facts["roll"], strict=True)(data)  # meant to be low
    assert not FallDetector.for_facts(humanoid, facts["crawl"], strict=True)(data)  # on hands and knees
    data.qpos[2] = 0.5
    assert not FallDetector.for_facts(humanoid, facts["walk"], strict=True)(data)


# ------------------------------------------------------------------------ the env
def start_from(env, data):
    env.reset(seed=0, options={"phase": 0.0, "state": env.layout.state_vector(data.qpos, data.qvel)})


def test_kneeling_ends_a_walk_episode_with_zero_reward(clips, humanoid):
    env = ImitationEnv(clips["walk"], EnvConfig(horizon_s=1.0), humanoid)
    start_from(env, on_the_floor(humanoid, kneeling(humanoid)))
    _, reward, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape))
    assert {"right_knee", "left_knee"} & touching(humanoid, env.data)
    assert terminated and not truncated and reward == 0.0
    # Without the zero-reward rule the same step is scored as usual (and is not zero).
    lenient = ImitationEnv(clips["walk"], EnvConfig(horizon_s=1.0, zero_reward_on_fall=False), humanoid)
    start_from(lenient, on_the_floor(humanoid, kneeling(humanoid)))
    _, reward, terminated, _, _ = lenient.step(np.zeros(lenient.action_space.shape))
    assert terminated and reward > 0.0


def test_ground_contact_links_config_lets_the_knees_down(clips, humanoid):
    config = EnvConfig(horizon_s=1.0, ground_contact_links=["right_knee", "left_knee"])
    assert config.ground_contact_links == ("right_knee", "left_knee")  # a list from JSON becomes a tuple
    env = ImitationEnv(clips["walk"], config, humanoid)
    start_from(env, on_the_floor(humanoid, kneeling(humanoid)))
    _, reward, terminated, _, _ = env.step(np.zeros(env.action_space.shape))
    assert touching(humanoid, env.data) <= FEET | {"right_knee", "left_knee"}
    assert not terminated and reward > 0.0
    with pytest.raises(ValueError, match="not links"):
        ImitationEnv(clips["walk"], EnvConfig(horizon_s=1.0, ground_contact_links=("knee",)), humanoid)


def test_a_hand_on_the_floor_mid_cartwheel_is_no_fall_under_its_rule_but_is_under_walks(clips, humanoid):
    """Mid-cartwheel (row 41: the right hand carries the body), playing the reference on:
    the cartwheel's rule lets the hand down, walk's rule (feet only) does not."""
    results = {}
    for rule in (None, ()):
        env = ImitationEnv(clips["cartwheel"], EnvConfig(horizon_s=1.0, ground_contact_links=rule), humanoid)
        _, info = env.reset(seed=0, options={"phase": float(env.track.phase[41])})
        assert info["start_step"] == 41
        _, reward, terminated, _, _ = env.step(np.zeros(env.action_space.shape))
        assert touching(humanoid, env.data) == {"right_wrist"}  # the same physics under either rule
        results[rule] = (terminated, reward)
    assert results[None][0] is False and results[None][1] > 0.8
    assert results[()] == (True, 0.0)


def test_roll_has_no_fall_rule(clips, humanoid):
    # The contact rule alone: a pose this far from the reference's also ends the episode by the
    # tracking termination (on by default), which is not what this test is about.
    env = ImitationEnv(clips["roll"], EnvConfig(horizon_s=1.0, sfv=SfvConfig(tracking_termination_m=0.0)), humanoid)
    start_from(env, on_the_floor(humanoid, head_down(humanoid)))
    touched = set()
    for _ in range(15):
        _, _, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape))
        assert not terminated and not truncated
        touched |= touching(humanoid, env.data)
    assert touched & {"root", "chest", "neck"}, "the torso or head did touch the floor"


def test_the_crawl_reference_is_no_strict_fall_anywhere_in_its_clip(humanoid):
    """Every frame of the crawl's own reference, posed with its contacts, passes the strict rule
    (its pelvis goes down to 0.17 m); a chest on the floor still fails it."""
    env = ImitationEnv(load_clip("crawl"), EnvConfig())
    strict = FallDetector.for_track(env.humanoid, env.track, strict=True)
    low = []
    for row in range(0, env.track.qpos.shape[0] // 10, 2):
        env.set_reference_state(row)
        mujoco.mj_forward(env.model, env.data)
        assert not strict(env.data), row
        low.append(env.data.qpos[2] < MIN_ROOT_HEIGHT)
    assert any(low)  # the floor would have fired
    down = on_the_floor(env.humanoid, head_down(env.humanoid))
    assert strict(down)
