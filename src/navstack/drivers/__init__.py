"""navstack.drivers."""
