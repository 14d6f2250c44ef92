"""Tracking experts, one per clip (NPMP, 004 §3.2): the training job over a clip list, the
mirrored experts that come by symmetry, and the expert table."""
