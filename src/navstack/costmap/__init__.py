"""navstack.costmap."""
