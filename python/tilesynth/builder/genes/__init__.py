"""The genes stage: where the sample patches come from (random and border-aware draws) and how a gene vector is
selected (GA/AIS and its objectives).
"""
