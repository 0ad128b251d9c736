"""navstack.navigation."""
