"""Core types: messages, SE(2) geometry, polygons, TF, errors, plugin registry."""
