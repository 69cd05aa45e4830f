"""Bad-input suite: malformed specs, scenes and CLI calls through the ``gearsym`` command."""
