"""The video-database benchmark's parts, one module each (``bench_videodb.py --part NAME``)."""
