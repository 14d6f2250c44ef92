"""What users take away from a run: the policy as ONNX, its motions as .npz and BVH."""
