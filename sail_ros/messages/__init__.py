"""The messages the project publishes and writes: one module per message, and its bytes.

Every message is exactly its CDR encoding, built in one place per message, for the
live simulator and the offline logs alike.
"""
