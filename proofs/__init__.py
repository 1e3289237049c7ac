"""The paper audit: one module per paper section, each claim a function returning a record."""
