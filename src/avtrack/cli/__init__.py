"""The ``avtrack`` command line."""
