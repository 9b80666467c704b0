"""The YAML tree language: its fields (`fields`), node kinds (`kinds`), the validator (`validator`,
`dataflow`), reading a file (`reader`), building the py_trees tree (`build`), substituting test
doubles (`substitution`, `doubles`), plug-ins (`plugins`), its JSON Schema (`schema`) and the
catalogue of skills and scenes (`catalogue`)."""
