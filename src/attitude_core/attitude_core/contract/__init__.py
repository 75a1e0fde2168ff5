"""The node contract: what crosses process boundaries, each defined once.

| module | defines |
|---|---|
| ``topics`` | topic names, message types, frames, stamps, QoS kinds |
| ``node_graph`` | the node table: package, executable, node name, topics, parameter table |
| ``status`` | ``PlannerStatus``: value, numeric code, diagnostic level |
| ``diagnostics`` | the planner's ``/diagnostics`` keys, written and parsed |
| ``exit_codes`` | the nodes' exit codes |
"""
