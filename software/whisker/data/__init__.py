"""Recorded and learned data: crash-safe recordings and their plots, whisker-contact datasets, and the
object classifier."""
