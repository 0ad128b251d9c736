"""navstack.control."""
