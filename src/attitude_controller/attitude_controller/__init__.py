"""PD attitude tracking controller node package."""
