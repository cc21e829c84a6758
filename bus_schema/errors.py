class SchemaError(ValueError):
    """A payload that does not match the schema; names the key and the field at fault."""

    def __init__(self, key: str, field: str, reason: str):
        self.key, self.field, self.reason = key, field, reason
        super().__init__(f"{key}: field {field!r}: {reason}")
