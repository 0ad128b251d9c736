"""User-facing interfaces: CLI, Python API, web dashboard, reports."""
