"""BehaviorTree.CPP v4 XML (the format Groot2 edits) both ways: `export_tree` writes a tree file
as XML, `import_xml` reads XML back into the YAML language; the mapping is docs/btcpp.md."""

from assembly.interop.btcpp.reader import import_xml
from assembly.interop.btcpp.writer import export_tree

__all__ = ["export_tree", "import_xml"]
