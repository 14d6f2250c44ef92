"""The character: the simulated body (MJCF, joints and their DoF addresses, PD gains and
torque limits, end effectors, links allowed on the ground, mirror map, reward joint weights),
its state vectors, kinematics and features. `humanoid3d` (DeepMimic's humanoid) is the first
`Character`."""
