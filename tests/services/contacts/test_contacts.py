"""The learned foot-contact estimator: features, synthetic training data, the shipped ONNX
model (checksum, accuracy on held-out clips and on the real Pose2Sim video), retraining."""
import shutil

import numpy as np
import pytest

from learner.errors import SfvError
from services.contacts.estimator import SHIPPED, FootContactEstimator, track_contacts
from services.contacts.features import FEATURES, WINDOW, frame_stride, window_features
from services.contacts.network import HIDDEN, contact_network
from services.contacts.settings import DIGEST_FILE, MODEL_FILE, REPORT_FILE, TrainSettings
from services.contacts.synthetic_data import (CONTACT_HEIGHT, FOOT_POINTS, HOLD_S, blazepose_like, held_poses, make_dataset,
                                              play_clip, random_camera_view)
from services.contacts.training import save_shipped, train_contact_network
from services.reconstruction.keypoints import FIT_NAMES

pytest.importorskip("pybullet_data", reason="the training clips come with pybullet_data")


def test_features_ignore_where_and_how_big_the_body_is_in_the_picture():
    rng = np.random.default_rng(0)
    points, confidence = rng.uniform(100, 300, (20, 17, 2)), rng.uniform(0, 1, (20, 17))
    features = window_features(points, confidence)
    assert features.shape == (20, FEATURES) and FEATURES == WINDOW * 17 * 3
    np.testing.assert_allclose(window_features(points * 1.7 + [40, -25], confidence), features, atol=1e-5)
    assert not np.allclose(window_features(points[::-1].copy(), confidence), features)
    assert frame_stride(60.0) == 2 and frame_stride(30.0) == 1 and frame_stride(24.0) == 1


def test_walking_labels_alternate_and_the_mirror_swaps_feet():
    walk, mirror = play_clip("walk")
    on = walk.contacts.mean(axis=0)
    assert ((on > 0.3) & (on < 0.8)).all()  # each foot is down for part of the gait, not always
    assert (walk.contacts.any(axis=1)).mean() > 0.9  # walking: almost always one foot down
    np.testing.assert_array_equal(mirror.contacts, walk.contacts[:, ::-1])
    pixels, in_front = random_camera_view(walk, np.random.default_rng(1), "tracking")
    assert in_front.all() and (pixels[..., 0] > 0).mean() > 0.9 and (pixels[..., 1] < 480).mean() > 0.9
    noisy, confidence = blazepose_like(pixels, np.random.default_rng(2))
    assert 0.01 < (confidence == 0).mean() < 0.1 and np.abs(noisy - pixels).mean() > 0.1


def test_held_poses_keep_a_foot_down_and_call_a_still_foot_down_only_when_it_is_low():
    holds = held_poses("walk", np.random.default_rng(3), count=4)
    assert len(holds) == 8 and all(len(h.points) == round(HOLD_S * 30) for h in holds)  # four and their mirrors
    for hold in holds:
        middle = len(hold.points) // 2
        assert hold.contacts[middle].any()  # chosen among the poses with a foot on the ground
        speed = np.linalg.norm(np.diff(hold.points[:, FOOT_POINTS, :2], axis=0), axis=-1).max() * 30
        assert speed < 0.6  # nearly still: what is down is decided by height alone
    lifted = [h for h in holds if not h.contacts[len(h.points) // 2].all()]
    assert lifted  # single support: some held poses have a foot in the air, labelled up though still
    for hold in lifted:
        up = int(np.flatnonzero(~hold.contacts[len(hold.points) // 2])[0])  # 0 right, 1 left
        ankle = FIT_NAMES.index("RAnkle" if up == 0 else "LAnkle")
        assert hold.points[len(hold.points) // 2, ankle, 2] > CONTACT_HEIGHT


def test_the_network_has_the_papers_layers():
    widths = [m.out_features for m in contact_network() if hasattr(m, "out_features")]
    norms = [m.num_features for m in contact_network() if m.__class__.__name__ == "BatchNorm1d"]
    assert widths == [*HIDDEN, 2] and norms == list(HIDDEN)


def test_the_shipped_model_is_checked_and_finds_contacts_on_held_out_clips(tmp_path):
    estimator = FootContactEstimator()
    data = make_dataset(("jump", "run"), cameras_per_clip=4, seed=123)  # clips the shipped model never saw
    probabilities = estimator._session.run(None, {estimator._input: data.features})[0]
    accuracy = ((probabilities > 0) == (data.labels > 0.5)).mean()
    assert accuracy > 0.8  # held-out accuracy of the shipped model: run 0.88, jump 0.90 (foot_contact.json)
    tampered = tmp_path / "weights"
    shutil.copytree(SHIPPED, tampered)
    with open(tampered / MODEL_FILE, "ab") as handle:
        handle.write(b"\0")
    with pytest.raises(SfvError, match=r"checksum .* does not match foot_contact\.sha256.*sfv contacts-train"):
        FootContactEstimator(tampered)


@pytest.mark.slow
def test_retraining_writes_a_model_whose_onnx_answers_like_torch(tmp_path):
    import onnxruntime as ort
    import torch

    settings = TrainSettings(epochs=1, cameras_per_clip=1, held_out=("kick",))
    network, report = train_contact_network(settings, log=lambda _: None)
    path = save_shipped(network, report, tmp_path)
    assert {p.name for p in tmp_path.iterdir()} == {MODEL_FILE, DIGEST_FILE, REPORT_FILE}
    assert set(report["held_out_accuracy"]) == {"kick"}
    features = make_dataset(("kick",), 1, seed=5).features[:50]
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    network.eval()
    with torch.no_grad():
        expected = network(torch.as_tensor(features)).numpy()
    np.testing.assert_allclose(session.run(None, {"windows": features})[0], expected, atol=1e-4)
    FootContactEstimator(tmp_path)  # its digest checks out


@pytest.mark.shared
def test_contacts_on_the_real_video_agree_with_the_markers(models_dir):
    from services.pose import estimate_video
    from tests.pose2sim_truth import CLIP_DIR, marker_contacts

    video = CLIP_DIR / "cam01.mp4"
    if not video.is_file():
        pytest.skip("../shared absent")
    track = estimate_video(video, models_dir=models_dir)
    probabilities, flags = track_contacts(track)
    assert probabilities.shape == flags.shape == (100, 2)
    truth = marker_contacts()
    accuracy = (flags == truth).mean(axis=0)
    # measured with the shipped model: 0.815 (cam02..04: 0.47, 0.895, 0.905); the model trained
    # without held poses scored 0.70 (0.55, 0.80, 0.87); always "down" scores 0.59
    assert accuracy.mean() > 0.75, f"right {accuracy[0]:.2f}, left {accuracy[1]:.2f}"


def test_contacts_train_refuses_an_unknown_held_out_clip(tmp_path, capsys):
    from services.cli import main

    assert main(["contacts-train", "--out", str(tmp_path / "net"), "--held-out", "run,jogging"]) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--held-out" in line and "jogging is not one" in line
    assert not (tmp_path / "net").exists()
