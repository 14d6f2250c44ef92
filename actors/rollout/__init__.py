"""Rollout: the workers that step envs with a policy and ship batches, and the ASI client."""
