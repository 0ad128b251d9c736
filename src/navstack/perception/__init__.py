"""navstack.perception."""
