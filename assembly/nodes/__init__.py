"""The py_trees behaviours the YAML language builds besides skills: sequence and selector, every
decorator (retry, repeat, inverter, timeout on the cell clock, guard, status map), conditions on
blackboard values and `for_each_element`, all ticking without generators under the runner."""
