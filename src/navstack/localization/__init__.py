"""navstack.localization."""
