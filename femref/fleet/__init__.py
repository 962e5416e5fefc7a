"""Fleets of measured recordings (docs/design.md §10): the manifest, the event store and the Dask runner."""
