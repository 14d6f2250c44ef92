"""Adaptive state initialization (SFV §7.1): a per-job learned initial-state distribution served over gRPC.

- distribution.py: the k-Gaussian distribution and its policy-gradient step (pure numpy)
- store.py / redis_store.py: where jobs live (in-process or Redis)
- server.py: the gRPC service, validation, auth, `serve` and `EmbeddedASIServer`
The client for rollout workers is actors/rollout/asi_client.py.
"""
