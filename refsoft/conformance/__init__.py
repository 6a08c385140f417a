"""Conformance for ports (spec section 8): the golden set (:mod:`.golden`), the rules that
judge a port's outputs against it (:mod:`.check`), and the float32 / float64 comparison behind
the tolerances (:mod:`.precision`)."""
