"""Synthesis: laying a tile set's tiles into an image of any size."""
