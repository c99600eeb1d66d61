"""The session core: one browser session's state, its motions, the one job runner and the rule for what the
viewer shows. It knows no tab: tabs (``app.tabs``) import it, never the other way round."""
