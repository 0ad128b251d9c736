"""navstack.planning."""
