"""Stages of the data flow that several schemes share (one home each).

* :mod:`~tilesynth.stages.compose`: the composed tile and its provenance (seam-weight gradients through the
  provenance, the exemplar record, the one :class:`~tilesynth.tilefile.TileSet` ending of every builder);
* :mod:`~tilesynth.stages.smoothing`: Poisson smoothing inside the cuts.

The other stages have their own top-level modules: :mod:`tilesynth.genes` (sample patches and the objective),
:mod:`tilesynth.select` (GA, AIS, best-of, polish), :mod:`tilesynth.matching` (matching-patch search),
:mod:`tilesynth.kernels` (cuts and the other Rust kernels), :mod:`tilesynth.tiling` (lookup),
:mod:`tilesynth.synthesis` (the image).
"""
