"""The Duet tab."""
