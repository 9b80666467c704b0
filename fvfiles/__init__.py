"""Files in and out, safely, for every package: the root of the errors a user can act on (each
naming its file, line and field), readers of YAML, XML and JSON that keep the line of every value
and refuse what could hurt, the check of values against the JSON Schema subset the formats use, and
writers that replace files atomically."""
