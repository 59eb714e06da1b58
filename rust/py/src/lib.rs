// binding: being written
