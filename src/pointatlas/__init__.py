"""pointatlas."""
