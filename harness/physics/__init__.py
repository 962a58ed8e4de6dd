"""The physics stage: what a log's own signals say about it. Wrong units from the redundancy every
chassis log has (``units``), quasi-steady stretches (``segments``), and opening a user's log the
way every command does, its units judged (``checked_log``)."""
