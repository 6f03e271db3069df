"""The built tile set (:class:`~tilesynth.tileset.tilefile.TileSet`) and its file format."""
