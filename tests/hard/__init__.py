"""Hard cases: extreme scales, grazing, chatter, chaos, long runs, simultaneous and moving surfaces."""
