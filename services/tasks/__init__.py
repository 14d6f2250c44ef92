"""Task policies on a frozen motor module (NPMP 004 §3.4): training, evaluation, videos."""
