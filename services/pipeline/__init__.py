"""The pipeline's finishing step: rollout from the first frame, report, pictures."""
