"""The C reference of the subloading return map (built on the fly; not part of the package)."""
