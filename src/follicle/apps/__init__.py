"""Applications built on the library: programs that compose grooming, formats and the
scene (the RenderMan procedural), kept out of the packages they use so no import runs
back up into them."""
