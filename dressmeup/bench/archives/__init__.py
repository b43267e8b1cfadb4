"""Archives of an edition's data parts: packing, fetching and verifying them (`archive`), the
bytes moved by a bounded read, a resumable download or a copy (`transfer`)."""
