"""The build pipeline of a tile set, stage by stage: options and masks, the genes (sample-patch draws, border-aware
draws, GA/AIS selection and its objectives), matching, the cut, composition, smoothing and map fusion; the ω and
Wang builders (:mod:`.omega`, :mod:`.wang`) orchestrate them and :mod:`.materials` extends them to material maps.
"""
