"""The rules of ``refsoft check``, one module per kind of rule (spec section 8): the G-buffer
(:mod:`.gbuffer`), the search (:mod:`.search`: reflection pixels, flags, iterations, scores,
traces), the virtual vertices (:mod:`.virtual`), the image and the ids (:mod:`.image`), the
layered depth textures (:mod:`.ldt` per pixel, :mod:`.ldt_texture` their textures) and the
environment map (:mod:`.envmap`); :mod:`.common` and :mod:`.perpixel` hold what they share.

Each rule module has the interface :mod:`refsoft.conformance.registry` lists; the registry
puts them in order. Nothing here imports the registry or the driver
(:mod:`refsoft.conformance.check`): imports go one way, driver -> registry -> rules.
"""
