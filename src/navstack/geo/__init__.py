"""navstack.geo."""
