"""A recording as the reference reader (the Python `mcap` package) sees it.

Usage: python3 read_cut.py FILE.mcap
Prints JSON: for the seeking reader (make_reader) and the streaming one
(NonSeekingReader), the messages read, the last log time and the error that
stopped it (null when it read to the end); the summary (null when the file
has none): its chunk indexes, its statistics' message count, and the
messages its indexes lead to.
"""

import json
import sys

from mcap.reader import NonSeekingReader, make_reader


def read(reader):
    messages, last, error = 0, 0, None
    try:
        for _, _, message in reader.iter_messages(log_time_order=False):
            messages += 1
            last = max(last, message.log_time)
    except Exception as e:  # what stopped the reader is the result
        error = f"{type(e).__name__}: {e}"
    return {"messages": messages, "last_log_time": last, "error": error}


def summary(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        s = reader.get_summary()
        if s is None:
            return None
        indexed = sum(1 for _ in reader.iter_messages())
        return {
            "chunk_indexes": len(s.chunk_indexes),
            "message_count": s.statistics.message_count if s.statistics else None,
            "indexed_messages": indexed,
        }


def main(path):
    with open(path, "rb") as f:
        seeking = read(make_reader(f))
    with open(path, "rb") as f:
        streaming = read(NonSeekingReader(f))
    try:
        s = summary(path)
    except Exception as e:
        s = {"error": f"{type(e).__name__}: {e}"}
    json.dump({"seeking": seeking, "streaming": streaming, "summary": s}, sys.stdout)


if __name__ == "__main__":
    main(sys.argv[1])
