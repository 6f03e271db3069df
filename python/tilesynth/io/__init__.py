"""Files in and out: images (PNG, EXR, 16-bit), normal-map encodings, and the one rule for the paths a command
touches.
"""
