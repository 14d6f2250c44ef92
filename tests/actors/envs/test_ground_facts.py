"""A clip's fall rule comes from its own reference (actors/envs/ground_facts.py, falls.py), not its
name: on DeepMimic's 15 clips the measured facts give DeepMimic's per-clip lists exactly (the
table this replaced), and a clip under another name gets the same rule."""
from __future__ import annotations

import dataclasses

import pytest

from actors.character.humanoid3d import HUMANOID3D
from actors.envs.falls import allowed_contact_links, goes_low, lies_on_the_ground
from actors.envs.ground_facts import GroundFacts, track_ground_facts
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from tests.conftest import load_clip

CLIPS = ("backflip", "cartwheel", "crawl", "dance_a", "dance_b", "getup_facedown", "getup_faceup", "jump", "kick",
         "punch", "roll", "run", "spin", "spinkick", "walk")
# The table the facts replace (DeepMimic's train args): extra links allowed, no fall rule, no height floor.
HANDS = {"right_wrist", "left_wrist"}
NO_FALL_CLIPS = {"roll", "getup_facedown", "getup_faceup"}
LOW_CLIPS = {"crawl"}
TORSO = {"root", "chest", "neck"}


def table_allowance(clip: str) -> set[str]:
    names = set(HUMANOID3D.link_names)
    if clip in NO_FALL_CLIPS:
        return names
    if clip == "crawl":
        return names - TORSO
    return set(HUMANOID3D.feet) | (HANDS if clip == "cartwheel" else set())


def clip_facts(clip: str, humanoid) -> GroundFacts:
    return track_ground_facts(humanoid, ImitationEnv(load_clip(clip), EnvConfig(), humanoid).track)


@pytest.mark.parametrize("clip", CLIPS)
def test_the_measured_facts_give_the_deepmimic_table(clip, shared_humanoid):
    facts = clip_facts(clip, shared_humanoid)
    assert set(allowed_contact_links(facts)) == table_allowance(clip)
    assert lies_on_the_ground(facts) == (clip in NO_FALL_CLIPS)
    assert (goes_low(facts) and not lies_on_the_ground(facts)) == (clip in LOW_CLIPS)


def test_a_cartwheel_under_another_name_gets_its_hands(shared_humanoid):
    renamed = dataclasses.replace(load_clip("cartwheel"), name="my_mocap_take_07", source="take_07.bvh")
    facts = track_ground_facts(shared_humanoid, ImitationEnv(renamed, EnvConfig(), shared_humanoid).track)
    assert HANDS <= set(allowed_contact_links(facts))
    env = ImitationEnv(renamed, EnvConfig(), shared_humanoid)
    allowed = set(HUMANOID3D.link_names) - {HUMANOID3D.link_names[i] for i in env.fall_detector.links}
    assert allowed == set(HUMANOID3D.feet) | HANDS


def test_an_upright_clip_allows_the_feet_only():
    assert set(allowed_contact_links(GroundFacts.upright(HUMANOID3D))) == set(HUMANOID3D.feet)
