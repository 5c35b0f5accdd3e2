"""visnav.app: assemble and run. A run built from a scenario (the navigator registry, the mission builders and
their parts, the one loop), the sessions around it (record, replay, SIL, bridge) and the campaigns. It is the one
package above ``sim``, ``io`` and ``analysis`` (docs/architecture.md, tests/test_import_rules.py)."""
