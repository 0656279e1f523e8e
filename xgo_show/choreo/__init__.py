"""choreo layer."""
