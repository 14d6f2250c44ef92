"""Task environments that reuse a motor module (NPMP 004 §3.4): go-to-target and push-box."""
