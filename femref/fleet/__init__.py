"""A fleet of recordings: the manifest, the event store and the gears' wear trends."""
