"""Arenas: what the character stands in (flat floor, boxes, push box)."""
