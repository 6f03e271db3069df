"""Layouts: which tile goes where. The papers' ω and Wang sets, the complete corner/edge sets, the scan-line tiler
and the hashed lookup.
"""
