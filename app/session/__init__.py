"""The session core: one browser session's state (``state.StudioState``), put together from one module per job:
its motions (``items``: a motion; ``motion_list``: the list and the motion library behind it), the one job runner
(``jobs``), the rule for what the viewer shows (``viewer_rule``), the Generate box and its jobs (``generation``),
counting the shown motion (``counting``) and duets (``duets``). It knows no tab: tabs (``app.tabs``) import it, never
the other way round."""
