"""The VEM multi-target tracking engine, target management, and the trackers built on it."""
