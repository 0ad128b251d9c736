"""navstack.missions."""
