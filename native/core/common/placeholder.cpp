// Translation unit anchoring the core library; domain code lives beside it.
