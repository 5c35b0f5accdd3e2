"""visnav: vision-based navigation, guidance and control for UAVs without GPS."""

__version__ = "0.1.0"
