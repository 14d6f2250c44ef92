"""Env modes: each bundles a reward, a termination and an observation for the env core."""
