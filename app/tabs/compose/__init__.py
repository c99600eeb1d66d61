"""The Compose tab."""
