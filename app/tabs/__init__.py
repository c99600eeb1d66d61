"""One package per tab of the studio: its settings (``settings.py``, a ``param.Parameterized`` held by the session),
its job (``job.py``, launched through ``StudioState.launch``) and its view (``view.py``). A tab imports the session
core, the engine, viz and the shared components, never another tab."""
