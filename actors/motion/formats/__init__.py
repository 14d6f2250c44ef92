"""Motion file formats: DeepMimic and the project's npz (`io`), BVH from any rig (`bvh*`,
`rigs`) and retargeting onto the character (`retarget`)."""
