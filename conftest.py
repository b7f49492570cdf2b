"""Repository-wide pytest configuration (doctests of the library run with the tests)."""

# fluidnb/widgets is a symlink to widgets/ (collected there); __main__ would run the CLI.
collect_ignore = ["fluidnb/widgets", "fluidnb/__main__.py", "dev.py", "binder", "notebooks"]
