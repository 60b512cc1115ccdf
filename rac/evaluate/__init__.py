"""``racc evaluate``: score diagnosis models against the faults injected into a run (§10.2)."""
