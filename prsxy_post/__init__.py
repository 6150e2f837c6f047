"""prsxy-post: an error-compensating post-processor for the PRS-XY hybrid machine tool."""

__version__ = "0.1.0"
