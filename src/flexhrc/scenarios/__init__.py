"""Ready-made scenarios: table assembly, IKEA kitchen, table setting, ball in a box."""
