"""Task run configs read back: a run saved before a setting existed keeps the behaviour it trained with."""
from services.tasks.config import TaskConfig


def test_a_run_saved_before_latent_directions_drives_the_whole_latent():
    saved = TaskConfig().to_dict()
    assert saved["env"]["latent_directions"] == 8  # today's default: the module's 8 principal directions
    del saved["env"]["latent_directions"]
    assert TaskConfig.from_dict(saved).env.latent_directions == 0
    saved["env"]["latent_directions"] = 4
    assert TaskConfig.from_dict(saved).env.latent_directions == 4
