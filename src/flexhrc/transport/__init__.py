"""Message transports: an in-process bus (default) and Zenoh for several processes or hosts."""
