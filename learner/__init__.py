"""The floor of sfv: PPO, networks, normalisation, checkpoints, the policy contract, errors.

Importing it sets `OMP_WAIT_POLICY=PASSIVE` (unless set already) before torch's OpenMP starts:
torch's threads otherwise spin while they wait for work, and on a machine shared with other
runs the spinning threads take the cores from the threads with work. Measured on 2 cores at
load average 14 (other trainings and pipelines running): one PPO update of 4096 samples took
7.8-22 s on 2 threads spinning, 0.54-1.33 s on 2 passive threads, 1.0-1.7 s on one thread.
"""
import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
