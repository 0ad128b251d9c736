"""Runtime: scheduler & clock, typed bus, lifecycle nodes, config loading, launch."""
