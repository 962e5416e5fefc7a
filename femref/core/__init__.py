"""The bottom layer: profiles, load signals, the resolved body, the time grid and the catalog of names.

Nothing here imports any other part of femref.
"""
