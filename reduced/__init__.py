"""Reduced models of freight-car impacts (numpy and scipy only; never imports femref)."""
