"""The sfv mode: DeepMimic/SFV imitation of the whole reference, root path included."""
