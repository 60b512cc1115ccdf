"""The loading layer: every file racc reads is read here, and every output directory written.

Engines (diagnosis, repair, observe, learn, synth, analysis, the board) take data and return
data; commands name files and call this package to turn them into that data.  See
docs/architecture.md.
"""
