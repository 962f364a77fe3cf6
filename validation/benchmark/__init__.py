"""``dualmech benchmark``: each engine's speed in positions per second (:mod:`.rows`) beside the compiled
closed-form yardstick of the slider crank (:mod:`.yardstick`), written as ``docs/performance.md``.  The
package imports none of them."""
