"""Sources for the pipeline: the one contract (:mod:`app.sources.contract`, light to import) and the sources that
fulfil it: the simulated room (:mod:`~app.sources.sim`), recordings (:mod:`~app.sources.recording`), live devices
(:mod:`~app.sources.live`); :func:`app.sources.open.open_source` opens one by name."""
