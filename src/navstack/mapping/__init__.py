"""navstack.mapping."""
