"""Reference motions: the clip (`reference_motion`), its per-control-step track
(`reference_track`), edits (`bend`) and the file formats it is read from (`formats/`)."""
