"""rtl_model."""
