"""The matching stage: the matching patch of each intermediate tile, its flip/rotate variants and the levers
against repetition (free cut region, diverse matching patches).
"""
