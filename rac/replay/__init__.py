"""Replay of recorded runs through the observers and the diagnosis engine (§6.4, §10.2).

``engine`` is transport-free: it takes observer specs, a diagnosis theory and a time-ordered
stream of observer inputs.  ``sources`` turns recordings and properties CSVs into that stream.
"""
