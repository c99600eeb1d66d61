"""The skeleton viewer: what it shows (scene.py) and its Panel view (view.py); the core decides what is shown."""
