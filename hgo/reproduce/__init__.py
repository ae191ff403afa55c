"""`hgo reproduce`: runs every registered paper figure and claim and writes the report."""
