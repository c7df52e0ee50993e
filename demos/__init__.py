"""The literate demos (a package, so that tests import them as ``demos.<name>``)."""
