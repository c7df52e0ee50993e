"""The stored small meshes (``*.msh``) and :mod:`meshes.generate`, which writes them."""
