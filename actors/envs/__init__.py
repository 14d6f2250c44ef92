"""The environments: one batched env core that steps, observes, rewards and ends episodes
(`vector_env`; the gymnasium env `imitation_env` is a batch of one), the modes that plug into it
(`modes/`: sfv, movingcam) and the task environments (`tasks/`)."""
